"""The lab: questions about the physics that the product's numbers raise, each answered by a controlled
experiment (not installed; ``ssskit`` never imports it). Which question each module answers, and where
its results are: ``experiments/README.md``.

* :mod:`.attribution` -- what each difference in the region table is (switch one cause off);
* :mod:`.variants` -- the scene variants those experiments render (backed, scaled, deepened);
* :mod:`.surface` -- Eq. 1 over the seen surface (the screen-space projection's share);
* :mod:`.thickness` -- a thin object's back losses (MCML's finite slab per pixel);
* :mod:`.oblique`, :mod:`.oblique_table`, :mod:`.flat` -- the light's and the camera's angles, the
  boundary and re-entry in the flat limit (MCML at oblique incidence; a flat medium at chosen angles);
* :mod:`.figure` -- the attribution's stored table and plot (``python experiments/region_attribution.py``).
"""
