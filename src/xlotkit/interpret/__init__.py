"""Interpretation of XLOT records: reading, segmentation, picks, stress."""
