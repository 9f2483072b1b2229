"""hapgate: golden models, tools and the command-line entry point of the hapgate project."""

__version__ = "0.1.0"
