"""The ``suspopt`` command line (``docs/commands.md``)."""

from suspopt.cli.main import main

__all__ = ['main']
