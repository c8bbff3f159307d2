"""Code generation: sympy expressions plus argument orderings → numerical
functions, with in-memory and on-disk caches.

Not built yet: filled by the code-generation work (see the project's issues).
It knows neither switching nor models.
"""
