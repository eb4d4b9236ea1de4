"""Linear float images: HDRImage, display mapping, OpenEXR/npy I/O."""
