"""MLflow "models from code" entry of the terrain model (no pickled Python object).

MLflow copies this file into the model and runs it when the model is loaded: it registers
an unconfigured :class:`terrain.serving.TerrainModel`, which reads its channels, window and
classes from the model's ``model_config`` in ``load_context``. Logging the model this way
avoids serializing a Python object with cloudpickle
(https://mlflow.org/docs/latest/ml/model/models-from-code/).
"""

from mlflow.models import set_model

from terrain.serving.pyfunc import TerrainModel

set_model(TerrainModel())
