"""One-off investigations, kept with their results (see README.md here)."""
