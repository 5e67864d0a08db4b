"""The objects a user builds a loop from: live controllers (:mod:`.controllers`), plants
(:mod:`.plants`), the loop's elements, sensor, actuator and disturbance
(:mod:`.elements`), and a plant's scheduled changes (:mod:`.schedule`). Of the rest of
:mod:`mfcontrol.api` they import only the translator :mod:`mfcontrol.api.params` (the live
``RecursiveIP`` fills its parameter column through it).
"""
