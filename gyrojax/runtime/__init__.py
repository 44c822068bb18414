"""How gyrojax runs its compiled code, in one place: the folder of its cache and JAX's persistent compilation cache
(:mod:`~gyrojax.runtime.cache`), its own traced functions kept across processes per argument shape
(:mod:`~gyrojax.runtime.kept`), and the threads it runs on (:mod:`~gyrojax.runtime.threads`).

The command line and a notebook or script that imports gyrojax get the same persistent compilation cache (a process
that chose its own keeps it); gyrojax's kept traces are saved and loaded beside it.
"""
