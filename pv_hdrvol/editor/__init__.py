"""The focus+context transfer-function editor (HDR VolVis section 5; issue 21, in
progress): the magnified data axis (:mod:`.axis`), the editor's model without a display
(:mod:`.model`) and ParaView's presets (:mod:`.presets`)."""
