"""fuzzynav's navigator (``--controller fuzzynav``), one concept per module.

:mod:`.controller` holds the design (its docstring), the decision
(``FuzzyNavController``, the stages of its step among its methods) and the factory;
:mod:`.blocks` its two fuzzy blocks merged and exported; :mod:`.memory` the perception
memory; :mod:`.planner` the bearing planner; :mod:`.tracker` moving obstacles and the
target; :mod:`.robot` the robot as it knows it; :mod:`.params`, :mod:`.parts` and
:mod:`.tuning` its crisp parameters, the parts that switch off and its tuning protocol.
"""
