"""The tool's own experiments, each one module declaring its jobs, its tables and its section, as a plugin's
experiment is (``pipeline.experiment.Experiment``); each is registered by one line of
``eval.report.experiments`` and switched by its key of the configuration's ``experiments`` (``pipeline.config``)."""
