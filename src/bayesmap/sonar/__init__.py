"""Specular-reading rejection for sonar rings (ICINCO 2007 fragment, SciTePress 16519, p. 494).

- :mod:`~bayesmap.sonar.bottom_up`: Acceptability and Agreeability;
- :mod:`~bayesmap.sonar.traits`, :mod:`~bayesmap.sonar.verification`: traits, Trait Verification;
- :mod:`~bayesmap.sonar.filter`: :class:`SpecularFilter`, the three stages as one stateful object;
- :mod:`~bayesmap.sonar.mapping`: grid mappers (eq. 1 cone model, Thrun ±0.4, ROS range layer);
- :mod:`~bayesmap.sonar.logs`: real plain-text logs; :mod:`~bayesmap.sonar.pipeline`: log → map.

See docs/sonar.md for every choice that fills the fragment's gaps.
"""
