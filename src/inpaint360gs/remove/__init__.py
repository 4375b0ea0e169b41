"""Click/id selection and removal of objects from the object-aware Gaussian field (paper Sec. 3.4).

* :mod:`.select` — what a click selects; :mod:`.config` — :class:`RemovalConfig`;
* :mod:`.geometry` — body, hull, hanging parts, footprint column on arrays of centres;
* :mod:`.objects` — :func:`remove_objects` (the removal steps) and :func:`fill_masks` (what is left to fill);
* :mod:`.stage` — the ``remove`` stage: folders in, ``removed/`` out.
"""
