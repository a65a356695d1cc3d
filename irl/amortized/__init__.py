"""An amortized posterior over a driver's parameters (DESIGN §22).

- :mod:`~drivestyle.irl.amortized.encoder`: an observed episode as the encoder reads it
  (``episode_features``, numpy) and the trajectory encoder (``build_encoder``, torch);
- :mod:`~drivestyle.irl.amortized.box`: the parameters' box and its logit map to
  unconstrained space;
- :mod:`~drivestyle.irl.amortized.estimator`: the neural posterior (the encoder and a zuko
  flow): sampling, densities and its verified file;
- :mod:`~drivestyle.irl.amortized.training`: its training on simulations (``train``);
- :mod:`~drivestyle.irl.amortized.calibration`: simulation-based calibration (SBC ranks,
  coverage of central intervals).

Needs the ``sbi`` extra (zuko, on torch) to train or load an estimator; importing this
package or any of its modules does not import torch.
"""
