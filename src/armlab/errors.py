"""Exceptions armlab raises on purpose; the CLI prints their one-line message, never a traceback."""


class ArmlabError(Exception):
    """Base class of every error armlab reports to a user (bad input, divergence, …)."""
