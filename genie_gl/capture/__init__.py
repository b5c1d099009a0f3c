"""The capture stage: rigs along trajectories (:mod:`.trajectory`) and the frames of a
mobile-scan map with its registration error (:mod:`.mobile_map`), composed around
``gg.capture`` (renderer, lens, plan, accuracy settings, effects)."""
