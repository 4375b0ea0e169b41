"""The browser viewer (``inpaint360gs view``; README "Viewer"): the trained 3DGS as Gaussian splats,
the training cameras with their photos, click to select the object to remove (the selection of
``inpaint360gs run --click``), run the removal with per-stage progress, compare before / removed /
inpainted.

:mod:`.session` holds what the page shows and does, without a web library (tests drive it
directly); :mod:`.app` puts it in the page with viser; :mod:`.server` starts viser's server
before anything heavy loads. The two import viser (an optional extra, ``pip install -e .[viewer]``)
inside functions."""
