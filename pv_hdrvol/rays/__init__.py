"""Cameras (and later lenses) as ray generators: ``camera.rays(size) -> Rays``."""
