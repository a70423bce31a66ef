"""The viewer room: the browser scene where people drive the robot and watch it think.

The app model, which knows nothing of the browser:

- :mod:`.model`        :class:`ViewerApp`: the world, the run, what a press does (its
  state and lock, and a method per user action, each done by one of its parts):
- :mod:`.driver`       the run and its simulation thread, the ``--rrd`` recording;
- :mod:`.history`      the run's history (the time slider) and results (label, metrics);
- :mod:`.editing`      the scenario and its edits (layout, obstacles, target, the editor);
- :mod:`.run_settings` what drives (controller, parts, geometry, perception, noise);
- :mod:`.teaching`     the inference shown (live, a past step, what-if mode);
- :mod:`.reading`      the snapshot the page draws from;
- :mod:`.state`        the records and limits they share (Snapshot, Ghost, ViewerError);

The viser side, one :class:`ViewerServer` per world, a coordinator of parts:

- :mod:`.server`       :class:`ViewerServer` (and a classroom tab's client-scoped surface);
- :mod:`.scene`        the robot, its beams and inputs, trails, ghost, ground and marks;
- :mod:`.handles`      the target's and the obstacles' drag handles;
- :mod:`.camera`       each tab's top-down camera, fitted to its canvas;
- :mod:`.controls`     the control panel (run, scenario, controller and sensing, view);
- :mod:`.status`       the status line, the message and the Result panel;
- :mod:`.plots`        the signal plots;
- :mod:`.inference_panel`  the Inference tab (rule viewer, firing strip, what-if mode);
- :mod:`.surface_panel`    the Surface tab (axes and held inputs, the operating point);
- :mod:`.editor_panel`     the Editor tab (membership sliders, download, reset);
- :mod:`.render`       the render loop, the one thread that draws;

The teaching views as pure functions, and the rest:

- :mod:`.views`        the inference view (term plots, summary), the teaching views' front;
- :mod:`.rule_table`   the rule table (rows, sticky headers, aggregated sets, centroids);
- :mod:`.surface_view` the control surface and the rule-firing strip as images;
- :mod:`.drawing`      what they draw with (Inference, sizes, colours, paths, sentences);
- :mod:`.editor`       the membership-function editor's layout;
- :mod:`.stepwise`     one inference taken apart, stage by stage;
- :mod:`.term_drag`    membership functions shaped by dragging their corners;
- :mod:`.starter`      a small two-input system to start a lesson with;
- :mod:`.lesson`       lesson files, saved from the page and opened again;
- :mod:`.classroom`    ``serve --classroom``: a world per tab, a teacher's push;
- :mod:`.guards`, :mod:`.origin_guard`  what the server takes from a browser;
- :mod:`.compat_viser` what the viewer reads of viser's internals, checked (version, names);
- :mod:`.budget`       what a browser can make the server keep (memory, ``--rrd``'s disk);
- :mod:`.serve`        the ``fuzzynav serve`` command.
"""
