"""The belief layer (paper §III, §IV-A, §V): where each concept lives.

- ``particles``: weighted-particle pose beliefs over supporting surfaces (:class:`PoseBelief`,
  :class:`Surface`), the observation model with false negatives and Gaussian noise
  (:class:`ObservationModel`), the Bayesian update with resampling and reinvigoration
  (:func:`update`);
- ``observation``: the belief streams' parameters (:class:`BeliefParameters`: eps, delta, the
  costs c and c', the observation model), hypothesised observations ``?obs = (z, X_i, eps)``
  (:func:`sample_obs`, the ``sample-obs`` stream of every shipped domain),
  visibility of a particle neighbourhood (:func:`visibility_mask`), the lower bound ``L_j`` and
  ``BVis`` (:func:`visibility_lower_bound`, :func:`bvis`), eq. 2
  (:func:`detection_probability_bound`), ``ObsCost`` (:func:`obs_cost`) and ``update-belief``
  (:func:`update_belief`);
- ``visibility``: batched PyBullet ray casts from a camera (:class:`PyBulletCamera`);
- ``determinize``: self-loop determinization ``c + c'/p - c'`` (paper §V-A);
- ``plot``: pictures of beliefs.

Submodules are imported on demand (``visibility`` needs PyBullet, ``plot`` matplotlib).
"""

from .determinize import self_loop_cost

__all__ = ["self_loop_cost"]
