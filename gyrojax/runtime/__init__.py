"""How gyrojax runs its compiled code, in one place: the folder of its cache and the process-wide compilation cache
of the command line (:mod:`~gyrojax.runtime.cache`), its own executables kept across processes per argument shape
(:mod:`~gyrojax.runtime.kept`), and the threads it runs on (:mod:`~gyrojax.runtime.threads`).

A notebook or script that imports gyrojax gets none of JAX's global settings but x64: gyrojax's kept functions are
saved and loaded by gyrojax itself; JAX's persistent compilation cache is switched on only in the command line's own
process, where every compiled function is gyrojax's.
"""
