"""CoMBiNa's filters (Maestrini et al., JGCD 2023): translational UKF, attitude/inertia UKF, axisymmetric fall-back.

* :mod:`estimators.combina.translation` — translational UKF in LVLH (§IV.A);
* :mod:`estimators.combina.attitude` — attitude and inertia-ratio UKF (§IV.B, eqs 25–32);
* :mod:`estimators.combina.acquisition` — the batch (MAP) start of that UKF from its first measured attitudes;
* :mod:`estimators.combina.axisymmetric` — the axisymmetric mode (§V.A, eqs 35–46);
* :mod:`estimators.combina.symmetry` — symmetry detection (§V, eq. 34) and the roll self-registration test;
* :mod:`estimators.combina.gates` — their measurement gates;
* :mod:`estimators.combina.unscented` — the unscented core they share.

The closed loop that drives them over a measurement sequence is :func:`studies.sim.combina.run_combina`.

References
----------
.. [1] Maestrini, De Luca, Di Lizia, *Relative Navigation Strategy About Unknown and Uncooperative
   Targets*, Journal of Guidance, Control, and Dynamics, 2023.
.. [2] Crassidis, Markley, *Unscented filtering for spacecraft attitude estimation*, JGCD 26(4), 2003.
"""
