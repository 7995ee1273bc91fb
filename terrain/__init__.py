"""terrain: let field robots feel the ground they drive on.

State estimation and wheel slip, terrain classification from proprioceptive signals,
desired-slip traction control and wheel-terrain simulation. See ``README.md`` (sections
"Layout" and "Where each equation lives") for the architecture; the one-way import layers
are the import-linter contract in ``pyproject.toml``.
"""

__version__ = "0.1.0"
