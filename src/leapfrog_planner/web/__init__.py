"""``leapfrog serve``: plan interactively in the browser.

:mod:`.schema` reads and checks requests (the scenario parser's own messages), :mod:`.pool` runs
the solves in worker processes (a bounded queue, a time limit per solve), :mod:`.worker` is what
those processes run, :mod:`.view` turns a result into what the page draws, and :mod:`.app` is
the Starlette application: the page (``static/``) and its JSON API.
"""
