"""The names and defaults that ``lcnav run``'s, ``study``'s, ``combina``'s and ``demo``'s options list in their help, as literals.

Importing the libraries that define them (:mod:`estimators.navigation`, :mod:`estimators.tuning`,
:mod:`studies.engine.registry`, ...) pulls in numba, SciPy, pandas and every study: ``lcnav run --help`` and a
misspelt option of ``run`` took ~8 s, ``lcnav study --help`` 4.6 s (issue 30). Each value here is the library's,
copied; ``tests/studies/test_interrupts_and_faults.py`` checks that they are equal, so a change in a library that is
not made here fails a test instead of showing a stale help text.
"""

from __future__ import annotations

#: Navigation filters (keys of :data:`estimators.navigation.FILTERS`).
FILTERS = ("ekf", "ukf")
#: Uses of a spin prior (:data:`studies.sim.navigation.PRIOR_USES`).
PRIOR_USES = ("none", "init", "proxy")
#: When the prior's proxy measurement is pushed (:data:`estimators.prior.PROXY_MODES`).
PROXY_MODES = ("always", "on_reject")
#: Named filter tunings (keys of :data:`estimators.tuning.TUNINGS`) and the default per truth physics
#: (:data:`estimators.tuning.DEFAULT_TUNINGS`).
TUNINGS = ("consistent", "settled", "relinearized", "general-conservative", "sc1-paper", "sc2-paper", "sc3-paper", "sc4-paper",
           "budgeted", "fixed-lag", "fixed-lag-torque-free", "sc1-conservative", "sc2-conservative", "sc3-conservative", "sc4-conservative")
DEFAULT_TUNINGS = {"torque-free": "fixed-lag-torque-free", "perturbed": "fixed-lag"}
#: Pose noise models (:data:`estimators.measurement.NOISE_MODELS`) and the defaults of :class:`estimators.measurement.PoseNoise`:
#: model, attitude amplitude (rad), position amplitude (m).
NOISE_MODELS = ("gaussian", "isotropic")
POSE_NOISE_MODEL = "gaussian"
POSE_SIGMA_Q_RAD = 0.12
POSE_SIGMA_R_M = 0.37
#: Truth physics (:data:`estimators.perturbations.TRUTH_PHYSICS`).
TRUTH_PHYSICS = ("torque-free", "perturbed")
#: Registered studies (keys of :data:`studies.engine.registry.STUDIES`).
STUDIES = ("truth", "tuning", "init", "proxy", "chain", "combina", "coverage", "timing")
#: How long a ``--scheduler`` has to answer by default, and at most, s (:data:`studies.engine.sweep.CONNECT_TIMEOUT_S`,
#: :data:`studies.engine.sweep.MAX_CONNECT_TIMEOUT_S`).
CONNECT_TIMEOUT_S = 20.0
MAX_CONNECT_TIMEOUT_S = 600.0
#: CoMBiNa's targets and the meshes that stand for them (:data:`studies.sim.combina.MESH_TARGETS`), and its pose sources
#: (:data:`studies.sim.combina.SOURCES`).
COMBINA_MESH_TARGETS = {"asymmetric": "box-wing", "symmetric": "atlas-centaur"}
COMBINA_SOURCES = ("simulated", "rendered")
#: Where ``lcnav demo`` writes by default (:data:`studies.catalog.demo.DEFAULT_OUT`).
DEMO_OUT = "runs/demo"
