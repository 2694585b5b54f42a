"""Plots of profiles and of drives (matplotlib)."""
