"""How gyrojax runs its compiled code, in one place: the folder of its cache and JAX's persistent compilation cache
for the command's process (:mod:`~gyrojax.runtime.cache`), its own compiled functions kept across processes per
argument shape (:mod:`~gyrojax.runtime.kept`, with the LAPACK kernels they call made ready,
:mod:`~gyrojax.runtime.lapack`), a record's rows in chunks of one size so that those shapes are few
(:mod:`~gyrojax.runtime.rows`), and the threads it runs on (:mod:`~gyrojax.runtime.threads`).

The command line and a notebook or script that imports gyrojax load the same kept executables; JAX's persistent cache,
a setting of the whole process, is turned on by the command alone.
"""
