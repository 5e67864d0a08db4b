"""What stands between the controller and the plant in a real loop: the sensor (noise,
quantisation, delay), the actuator (delay, rate limit) and the disturbance, each a small
pure function over floats that the compiled engine composes around the law and the plant
(:mod:`mfcontrol.engine.compose`); :mod:`.layout` lays their parameters out in one column
per member."""
