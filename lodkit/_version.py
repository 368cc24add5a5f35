"""lodkit's version, in one module every other one can import without a circle."""

__version__ = "0.1.0"
