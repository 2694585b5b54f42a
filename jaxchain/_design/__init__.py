"""Tooth-profile design: the design space and the objectives."""
