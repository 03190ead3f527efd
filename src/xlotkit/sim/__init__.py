"""Simulation of XLOTs: lumped model and 2D hydro-mechanical MDEM model."""
