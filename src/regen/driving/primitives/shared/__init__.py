"""What several primitives share: lanes and lane changes, a lead vehicle's braking, junction
paths, state switches, and a driver's attention at a light. Not primitives themselves: the
registry reads only the modules beside this package.
"""
