"""Pure numpy/scipy numerical core of drake_dynid.

Nothing in this package imports Drake's Python bindings (a test enforces it).
Design functions return immutable data; step functions take state and return new
state, so the same code serves the Drake blocks, the log replay and the benchmarks.
The on-line identifier's core is ``online`` (settings, timing, results),
``identifier`` (the solve step) and ``replay`` (the whole log at once); the
README's Layout section maps every module.
"""
