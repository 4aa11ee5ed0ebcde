"""Figures of tactile files (matplotlib, headless)."""
