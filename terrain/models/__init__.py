"""Terrain classifiers (SVM, CNN), run-grouped cross-validation and metrics."""
