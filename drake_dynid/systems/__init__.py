"""Drake ``LeafSystem`` blocks of drake_dynid.

Each block is a thin wrapper over ``drake_dynid.core``: it declares ports, keeps all
of its state in the Context and calls the core step functions.

The blocks are double-only Python systems: ``ToAutoDiffXd``/``ToSymbolic`` and
``System.Clone()`` (hence ``copy.deepcopy`` of a system) raise Drake's message that
the system has no scalar conversion. Contexts clone and reset as usual
(``context.Clone()``, ``SetDefaultContext``): two Contexts of one diagram never
share state. Every stateful block declares its periodic update as a forced event
too (as Drake's ``DiscreteDerivative``): ``ExecuteForcedEvents(context)`` runs one
update with the inputs as fixed, for unit tests without a Simulator.
"""
