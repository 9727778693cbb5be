"""Estimators: attitude maths, dynamics, the EKF and UKF of Renis et al. [1]_ and the CoMBiNa filters of Maestrini et al. [2]_.

Notebook use: build a filter from a named tuning and step it with ``predict`` and ``update``
(:mod:`estimators.ekf`, :mod:`estimators.ukf`); the CoMBiNa filters are
:mod:`estimators.combina.translation`, :mod:`estimators.combina.attitude` and
:mod:`estimators.combina.axisymmetric`. :mod:`estimators.attitude` holds the
attitude maths every package shares (pure functions, no state).

References
----------
.. [1] Renis, Price, Hellmich, Battipede, Salzmann, *Leveraging Light-Curve Inversion for Real-Time
   Kinematic State Estimation of Uncooperative Targets*.
.. [2] Maestrini, De Luca, Di Lizia, *Relative Navigation Strategy About Unknown and Uncooperative
   Targets*, Journal of Guidance, Control, and Dynamics, 2023.
"""
