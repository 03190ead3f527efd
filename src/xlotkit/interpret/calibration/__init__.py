"""Calibration of the pick intervals on constructed records with a known truth.

Submodules
----------
records
    A small generator of XLOT records by construction (well storage, a fracture whose
    compliance leaves the system over a smooth transition around a known closure pressure,
    several leak-off models, a choke flowback, gauge noise, sample interval and
    quantisation), each with its truth.
study
    Draw many records, pick them with the toolkit's own pipeline and measure how often
    each pick's nominal interval contains the truth, and how wide it is.
"""
