"""``inpaint360gs run``: the stages of the method in order on one scene (paper Alg. 1)."""
