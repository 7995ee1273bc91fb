"""terrain: let field robots feel the ground they drive on.

State estimation and wheel slip, terrain classification from proprioceptive signals,
desired-slip traction control and wheel-terrain simulation. See ``README.md`` and
``DESIGN.md`` (in the shared folder) for the architecture.
"""

__version__ = "0.1.0"
