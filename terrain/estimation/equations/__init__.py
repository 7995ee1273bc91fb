"""The equations of the EKF models, each written once as a pure, numba-compiled function.

One module per vehicle, in the explicit style of python-control's ``NonlinearIOSystem``:

* ``f(x, u, dt, params) -> x_next`` (process model), ``F(x, u, dt, params)`` (its Jacobian),
* ``h(x, params) -> z`` (measurement model), ``H(x, params)`` (its Jacobian),

with ``params`` a frozen, cited parameter dataclass. Underneath, each model is one pair of
in-place kernels ``transition_into(x, u, dt, p, fx, F)`` and ``observation_into(x, p, hx, H)``
(``p`` = the dataclass packed as a float array, :meth:`as_array`); ``f``/``F``/``h``/``H``,
the NumPy model classes of :mod:`terrain.estimation` (through
:class:`terrain.estimation.model.KernelModel` and :mod:`.evaluate`) and the compiled loop of
:mod:`terrain.estimation.fast` all call these same kernels. The vehicle kinematics inside
them (rigid-body point velocity, wheel rim speed, skid-steer side speeds) are not written
here: they are the ``register_jitable`` functions of :mod:`terrain.vehicles`, inlined.

* :mod:`.agrimaro`: the AgriMaRo 12-state design (seed ``001_59da564c4b2d6a48.txt`` ch. 6.1,
  eqs. 6.2, 4.33-4.34, 6.6) and the 14-state slip-in-state design (ch. 4.3, eqs. 4.20, 4.22,
  4.26-4.28, 4.36);
* :mod:`.skid_steer`: the 4-state skid-steer model (ICR factor, seed ``000_f24201ff985633bf.txt``
  eq. 3 and Mandow et al. 2007).
"""
