"""Visibility culling with plenoptic opacity functions (Gao et al. 2003)."""
