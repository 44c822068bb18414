"""The physics, pure and jit/vmap/grad-safe: site frames (Earth rate, gravity; :mod:`~gyrojax.physics.frames`),
the turntable's gimbal chain (:mod:`~gyrojax.physics.kinematics`), the named-effect registry and its built-ins
(:mod:`~gyrojax.physics.registry`, :mod:`~gyrojax.physics.effects`) and the one measurement model used by
simulation, fitting, diagnosis and design (:mod:`~gyrojax.physics.model`)."""
