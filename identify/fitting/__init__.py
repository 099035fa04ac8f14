"""fitting: the collision model fitted to a measurement, with its uncertainty.

    measurement ──wheel_spin──▶ the samples the model can follow
        ──model──▶ free parameters (transforms, priors of measured facts) and sim.Params
        ──collision_fit.fit──▶ FitResult: values, covariance (least_squares), identifiability,
                               at-bound and pull checks, the model's own error (model_error)
        ──residuals──▶ where the residuals stop looking like measurement noise

- ``wheel_spin``: wheel channels fitted only while the wheel rolls (a spinning wheel is left out).
- ``model``: what the fit moves (``FreeParameter``) and how values become the simulation's inputs.
- ``least_squares``: residual rows, correlation time and covariance, independent of the crash model.
- ``collision_fit``: ``fit(measurement, vehicle, ...) -> FitResult``, multi-start Levenberg-Marquardt.
- ``model_error``: the model-form standard deviation, calibrated on the reference world
  (``model_error.json``), added to every fitted standard deviation.
- ``residuals``: whiteness and bias of each channel's residual (discovery's trigger).
"""
