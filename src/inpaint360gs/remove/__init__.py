"""Click/id selection and removal of objects from the object-aware Gaussian field (paper Sec. 3.4)."""
