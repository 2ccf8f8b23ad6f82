"""The SMR predictor (SPEC 7): the estimator, its training on the pooled train splits, the per-attribute and
leave-one-method-out predictors, and the frame ranges each was trained on."""

from vpr_smr.eval.predictor.estimator import SMRPredictor

__all__ = ["SMRPredictor"]
