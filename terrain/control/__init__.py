"""Traction control: the desired-slip table and the traction PID (seed 001 ch. 8.2-8.3)."""
