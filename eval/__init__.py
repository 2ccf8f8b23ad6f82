"""Everything after the descriptors, one room per stage of the data flow (imports run down this list):

- ``report``: tables, figures and ``report.html`` of a run;
- ``scoring``: precision-recall curves, match removal and restoration, the evaluation of a method, held-out scores;
- ``predictor``: the SMR predictor (estimator), its training, the attribute and leave-one-method-out predictors;
- ``matching``: distance matrices, sequence matching, attributes and labels, compiled kernels, the live API.
"""
