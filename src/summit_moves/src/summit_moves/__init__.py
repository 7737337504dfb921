"""Scripted paths for the ground vehicle carrying the landing pad."""
