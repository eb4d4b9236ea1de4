"""Sort-last parallel rendering on MPI (Gao et al. 2003, section 4): blocks dealt to
ranks along a space-filling curve, each rank rendering only its visible blocks,
premultiplied float partial images composited by direct send over image tiles."""
