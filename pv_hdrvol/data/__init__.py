"""Datasets to flat arrays: image volumes and transfer-function tables."""
