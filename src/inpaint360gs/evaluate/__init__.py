"""The evaluation stage: scores of a method's result (against ground truth, or without it on real captures)."""
