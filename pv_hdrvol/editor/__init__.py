"""The focus+context transfer-function editor (HDR VolVis section 5; issue 21, in
progress): the magnified data axis so far."""
