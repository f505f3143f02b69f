"""Gravity-aided navigation on the vehicle computer: the bound, the planner, SITAN (wang2023)."""
