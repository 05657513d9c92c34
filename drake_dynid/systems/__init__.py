"""Drake ``LeafSystem`` blocks of drake_dynid.

Each block is a thin wrapper over ``drake_dynid.core``: it declares ports, keeps all
of its state in the Context and calls the core step functions.
"""
