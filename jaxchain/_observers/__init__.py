"""Observers: quantities computed along the one solve (peaks, soft peaks, order spectra,
engagements)."""
