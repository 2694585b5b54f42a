"""Design-optimization runs for jaxchain (``python -m optimize``)."""
