"""Interactive exploration (issue 21, in progress): progressive refinement with
cancellation (:mod:`.progressive`)."""
