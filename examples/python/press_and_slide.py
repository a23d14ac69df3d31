"""Press the TacTip onto the square's edge, slide 3 mm along it, show both images.

    pip install ./python matplotlib && python examples/python/press_and_slide.py
"""

import matplotlib.pyplot as plt

import tacsim

contact = tacsim.Contact(tacsim.Sensor.load(), tacsim.Scene("square"), max_depth_mm=2.0)  # grid for presses up to 2 mm
contact.press((45.0, 0.0, 1.5, 0.0))  # x, y (mm), depth (mm), yaw (deg): on the right edge
pressed = contact.image(256)
print("pressed: force (N)", contact.force_n.round(3))
contact.slide_to((45.0, 3.0, 1.5, 0.0), step_mm=0.25)  # stick/slip history kept
print("slid:    force (N)", contact.force_n.round(3), "cells in contact, slipping", contact.contact_cells)
fig, ax = plt.subplots(1, 2, figsize=(8, 4))
for a, img, title in zip(ax, [pressed, contact.image(256)], ["pressed", "slid 3 mm along the edge"]):
    a.imshow(img, cmap="gray")
    a.set_title(title)
    a.axis("off")
plt.show()
