"""Ray marching and HDR compositing."""
