"""Apps a user runs on their own data: the demo, recording a demonstration, teleoperation.

Reproducible studies (Table 5.1 and its variants) are in :mod:`dexlfd.experiments`;
both run batches on :mod:`dexlfd.engine`.
"""
