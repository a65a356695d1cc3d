"""An amortized posterior over a driver's parameters (DESIGN §22).

- :mod:`~drivestyle.irl.amortized.encoder`: an observed episode as the encoder reads it
  (``episode_features``, numpy) and the trajectory encoder (``build_encoder``, torch);
- :mod:`~drivestyle.irl.amortized.box`: the parameters' box and its logit map to
  unconstrained space;
- :mod:`~drivestyle.irl.amortized.estimator`: the neural posterior (the encoder and a zuko
  flow): sampling, densities and its verified file;
- :mod:`~drivestyle.irl.amortized.training`: its training on simulations (``train``);
- :mod:`~drivestyle.irl.amortized.calibration`: simulation-based calibration (SBC ranks,
  coverage of central intervals);
- :mod:`~drivestyle.irl.amortized.simulations`, :mod:`~drivestyle.irl.amortized.evaluation`:
  its training data from the stochastic driver, its held-out evaluation;
- :mod:`~drivestyle.irl.amortized.identify`: an episode observed up to any sample
  identified by it (``identify_amortized``, ``AmortizedStyle``), and a command's
  ``--posterior FILE`` (``open_posterior``);
- :mod:`~drivestyle.irl.amortized.tracker`: its online form (``AmortizedTracker``: one GRU
  step per sample);
- :mod:`~drivestyle.irl.amortized.mining`: ``mine-styles --posterior``'s ``amortized.csv``.

Needs the ``sbi`` extra (zuko, on torch) to train or load an estimator; importing this
package or any of its modules does not import torch.
"""
