"""startrack: a star-tracker simulator and star-identification bench."""

__version__ = "0.1.0"
