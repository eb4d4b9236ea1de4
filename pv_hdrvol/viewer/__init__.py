"""Interactive exploration (docs/interactive.md): progressive refinement with
cancellation (:mod:`.progressive`), HDR volumes in PyVista scenes (:mod:`.scene`,
``plotter.hdrvol``), the Qt viewer (:mod:`.qt`) and the notebook editor
(:mod:`.notebook`). Qt, PyVista and ipywidgets are imported only by the modules
that need them."""
