"""Values on an MQTT broker as a linkview source (aiomqtt), and a broker for its mock."""

from .broker import Mosquitto, mosquitto_binary
from .connector import MqttConnector, MqttSettings, NoMessageYet
from .nodes import Node, PayloadError, check_mqtt_url, mqtt_address, parse_node, value_in
from .publisher import MachinePublisher, document, payloads

__all__ = [
    "MachinePublisher",
    "Mosquitto",
    "MqttConnector",
    "MqttSettings",
    "NoMessageYet",
    "Node",
    "PayloadError",
    "check_mqtt_url",
    "document",
    "mosquitto_binary",
    "mqtt_address",
    "parse_node",
    "payloads",
    "value_in",
]
