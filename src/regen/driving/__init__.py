"""Driving domain: generated OpenDRIVE maps, Scenic (Newtonian) simulation, grounding with CP-SAT.

Heavy imports (scenic, scenariogeneration, ortools) happen inside the modules that need them.
"""
