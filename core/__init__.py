"""Shared helpers at the bottom of the data flow: atomic file writes with provenance, constants, output paths, and
the one codec of the result records (``core.records``).

Every other package may import these; they import nothing of the project's own.
"""
