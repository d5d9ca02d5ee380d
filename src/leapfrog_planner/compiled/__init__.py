"""The compiled core: the numba code generated per vehicle model, and what it exchanges with
Python.

- ``codegen.py`` prints a model's canonical system as numba code, followed by the kernel
  templates ``flow_template.py`` (the Runge-Kutta integrator) and ``newton_template.py`` (the
  Newton loops); ``linear.py`` is the small linear algebra that they and the Python loop share.
- ``abi.py`` declares the typed records of the kernels' arguments and results, ``status.py``
  the status codes.
- ``kernels.py`` caches the generated module on disk per model and loads it (``cache_key.py``
  computes its key from the files that feed it), and gives a kernel's entry point for callers
  that call it many times with arguments of fixed types.

It comes after the symbolic model (``model/``) and before everything numerical: nothing here
imports ``integrate``, ``roots`` or ``bvp``. Nothing is imported here, so that importing one
module (the status codes) does not load numba.
"""
