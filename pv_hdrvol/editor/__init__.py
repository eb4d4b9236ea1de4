"""The focus+context transfer-function editor (HDR VolVis section 5), without a
display: the magnified data axis and the value axes (:mod:`.axis`), the edited model
(:mod:`.model`) and ParaView's presets (:mod:`.presets`). The Qt and notebook widgets
over the model live in :mod:`pv_hdrvol.viewer`."""
