"""Scoring (method §§8-9): precision-recall curves and their areas, match removal and restoration, the evaluation of a
method on its evaluation splits, and the held-out method's scores under the leave-one-method-out predictor."""
