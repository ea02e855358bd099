"""Where the package's files live and how it reads and writes them: the shipped configs' paths,
outputs written only where asked, a run's files, JSON and CSV read with limits, policy specs as
directory names."""
