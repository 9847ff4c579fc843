"""crandall: a body sliding with Coulomb friction on a white-noise-shaken foundation.

Exact-in-law simulation (C++ core) and the analytic results of Berezin & Zayats.
"""
