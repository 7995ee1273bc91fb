"""MLflow "models from code" entry of the served streaming model (no pickled object).

MLflow copies this file into the model and runs it when loading: it registers an
unconfigured :class:`terrain.serving.served.ServedStreamModel`, which reads its settings
from the model's ``model_config`` in ``load_context``.
"""

from mlflow.models import set_model

from terrain.serving.served import ServedStreamModel

set_model(ServedStreamModel())
