"""The interactive viewer (`lift-gl view`): a thin layer over Renderer.

| module              | concern                                                        |
| ------------------- | -------------------------------------------------------------- |
| command.py          | the `view` subcommand (argparse); imports nothing heavy        |
| window.py           | the window, input events, the frame loop, scripted screenshots |
| session.py          | the viewer's state over the Renderer, testable without a window |
| camera_controller.py| fly and orbit navigation (numpy)                               |
| bookmarks.py        | camera bookmarks beside the scene (TOML)                       |
| image_view.py       | draws the display texture (and the split view) into the window |
| aov_view.py         | G-buffer channels as display colours                           |
| scene_catalog.py    | the scenes the scene picker lists                              |
| imgui_renderer.py   | ImGui drawing (moderngl-window's integration, two fixes)       |
| panels/             | one module per GUI panel                                       |

Only command.py is imported by `lift-gl` itself; moderngl-window and imgui-bundle load when
the viewer starts.
"""
