"""The package's version: a leaf, so that the writers can name it without importing the API."""

__version__ = "0.1.0"
