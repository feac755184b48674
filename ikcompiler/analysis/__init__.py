"""Analysis of a loaded chain: Jacobians, manipulability measures and singular configurations (issue 12).

``jacobian`` (numeric, vectorised), ``symbolic`` (exact sympy Jacobians), ``singularities`` (the singular
set: symbolic conditions confirmed by sampling), ``plot`` (PNG figures), ``cli`` (``ikc singularities``).
"""
