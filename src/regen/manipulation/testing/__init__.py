"""Policy testing in manipulation: a user's policy drives the Franka Panda of a verified
scenario in PyBullet, in place of the scripted motion primitives.

Modules: ``types`` (the observation and action a policy sees and returns, with units and
limits), ``policies`` (the built-in ``scripted``, ``random`` and ``sac`` policies and
:func:`~regen.manipulation.testing.policies.load_policy`), ``loop`` (the closed policy loop with
its per-step timeout and policy faults), ``variants`` (other CP-SAT placements of the context)
and ``harness`` (:class:`~regen.manipulation.testing.harness.ManipulationHarness`, the domain's
:class:`regen.harness.contract.PolicyHarness`: oracle stages, incidents, template check,
failure pictures).

Imports: every lower manipulation stage (world up to render), ``regen.verify`` and the shared
harness contract and timeout; nothing imports this package but the backend and the gym env.
"""
