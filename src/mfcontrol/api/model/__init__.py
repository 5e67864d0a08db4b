"""The objects a user builds a loop from: live controllers (:mod:`.controllers`), plants
(:mod:`.plants`) and the loop's elements, sensor, actuator and disturbance
(:mod:`.elements`).
"""
