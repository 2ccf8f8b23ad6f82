"""The SMR predictor (method §7): the estimator (``estimator.SMRPredictor``), its training on the pooled train
splits, the per-attribute and leave-one-method-out predictors, and the frame ranges each was trained on.

Nothing is imported here, so that ``defaults`` loads without scikit-learn."""
