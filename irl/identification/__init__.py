"""Identifying styles: which risk a demonstration was driven with, offline, online, at scale.

- ``library``: style libraries by risk (the driver library and the paper model's), their file
  and learning one.
- ``posterior``: the posterior over the risk (``identify`` → ``Identification``); the paper
  model's scorers (``paper_scorers``); what identification returns (``result``) and its
  verdict (``verdict``).
- ``online``: online identification, the posterior updated sample by sample.
- ``mining``, ``mined_row``, ``mining_output``: many vehicles, one row each (a row of
  ``styles.csv``), and a mining run's folder.
"""
