"""Reproducible studies: payload Table 5.1, its Monte-Carlo and Franka-protocol versions, lift."""
