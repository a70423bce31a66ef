"""The viewer room: the browser scene where people drive the robot and watch it think.

- :mod:`.model`        the app model (:class:`ViewerApp`): the world, the run, what a
  press does; it knows nothing of the browser;
- :mod:`.server`       the viser side: scene, panels and plots for each tab;
- :mod:`.views`        the teaching views as pure functions (inference, surface, rules);
- :mod:`.editor`       the membership-function editor's layout;
- :mod:`.classroom`    ``serve --classroom``: a world per tab, a teacher's push;
- :mod:`.guards`, :mod:`.origin_guard`  what the server takes from a browser;
- :mod:`.serve`        the ``fuzzynav serve`` command.
"""
