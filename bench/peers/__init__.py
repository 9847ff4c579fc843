"""Peers: Euler-Maruyama for the paper's eq3 written the way users write it (bench only)."""
