"""The residual rule of :func:`inpaint360gs.metrics.removal.view_counts` in closed form: the model's
depths are compared with the model's own depths before the removal, the true depths only say where
to judge, so a model whose depths are off the truth by more than the tolerance (a structure-from-motion
frame, floaters pulling the expected depth forward) is still scored right."""

import numpy as np
import pytest

from inpaint360gs.metrics.removal import DEPTH_TOLERANCE, view_counts

H, W = 8, 10


def _scene():
    fp = np.zeros((H, W), bool)
    fp[2:6, 3:7] = True  # the object: 16 pixels
    d_free = np.full((H, W), 2.0)  # the wall behind it
    d_with = np.where(fp, 1.5, d_free)  # the object 25 % in front of it
    d_with[2, 3:7] = 1.99  # its top row touches the wall: within the tolerance, not judged
    colour = np.full((H, W, 3), 0.5)
    return fp, d_with, d_free, colour


@pytest.mark.parametrize("bias", [1.0, 0.8, 0.95, 1.3])  # the model's depth per true depth
def test_residual_counts_what_still_shows_the_objects_surface_whatever_the_models_depth_bias(bias):
    fp, d_with, d_free, colour = _scene()
    alpha = np.ones((H, W))
    before = bias * d_with
    kept = view_counts(fp, d_with, d_free, before, before.copy(), alpha, colour, colour)  # nothing removed
    assert kept.residual == 12 and kept.footprint == 16  # every judged pixel (the 4 touching ones are not)
    revealed = bias * d_free  # the object gone, the wall behind it showing
    gone = view_counts(fp, d_with, d_free, before, revealed, alpha, colour, colour)
    assert gone.residual == 0
    # the object's surface moved by less than the tolerance (a refit) is still the object; by more, it is not
    near = view_counts(fp, d_with, d_free, before, before * (1 + 0.5 * DEPTH_TOLERANCE), alpha, colour, colour)
    far = view_counts(fp, d_with, d_free, before, before * (1 + 2 * DEPTH_TOLERANCE), alpha, colour, colour)
    assert (near.residual, far.residual) == (12, 0)
    # no surface left (alpha below one half): nothing stands there
    assert view_counts(fp, d_with, d_free, before, before.copy(), np.full((H, W), 0.4), colour, colour).residual == 0
