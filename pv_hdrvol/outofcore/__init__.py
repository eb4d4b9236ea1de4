"""Volumes larger than memory: multiresolution OME-Zarr stores and their out-of-core rendering."""
