"""Reproducible speed and accuracy measurements; each writes its section of docs/RESULTS.md."""
