"""Plots for XLOT records, picks and stress estimates (matplotlib, Agg backend)."""
