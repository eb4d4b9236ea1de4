"""Visualization by proxy: depth, multi-perspective and attenuation proxy images of a volume, explored without it."""
