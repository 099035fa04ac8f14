"""video: from a high-speed film of a frontal barrier test to the measured motion of the
car in metres and seconds, with an uncertainty per sample. Knows pixels and metres,
nothing about crash physics (never imports ``sim``)."""
