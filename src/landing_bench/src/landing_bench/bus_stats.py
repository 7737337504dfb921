"""What the nodes of a running graph say they published (their getBusStats over XML-RPC), ROS-free but for the
XML-RPC calls: how many messages each topic carried, from which the census of the messages delivered per sim
second (bench_loop) and the publication rates of the graph floor (graph_floor) are read. Sim seconds come from
the simulator's own /clock messages, so no clock subscription of ours is needed (nor counted)."""
import xmlrpc.client

SIMULATOR = "/mujoco_sim"
NODE_TIMEOUT_S = 5.0  # how long a node may take to answer an XML-RPC call [wall s]


def published_counts(bus_stats):
    """{topic: (connections, messages sent over them, most sent over one of them)} of one node's publications, from
    its XML-RPC getBusStats: rospy answers [code, text, stats] with [connection id, bytes, messages, connected] per
    connection, roscpp [stats] with [connection id, bytes, data bytes, messages, ...]. The oldest connection has
    carried every message since it was made: the last figure counts the topic's messages even when subscribers came
    and went."""
    stats = bus_stats[2] if isinstance(bus_stats[0], int) else bus_stats
    counts = {}
    for entry in stats[0]:
        topic, connections = entry[0], entry[-1]
        index = 3 if connections and len(connections[0]) >= 5 else 2
        sent = [c[index] for c in connections]
        counts[topic] = (len(connections), sum(sent), max(sent, default=0))
    return counts


def deliveries_per_sim_second(first, second, sim_seconds):
    """[(messages delivered per sim second, topic, publishing node, connections)], most first, from two census
    snapshots {node: {topic: published_counts}} taken ``sim_seconds`` apart (a connection made between them
    counts from zero)."""
    rows = []
    for node, topics in second.items():
        for topic, (connections, sent, _) in topics.items():
            before = first.get(node, {}).get(topic, (0, 0, 0))[1]
            if sent > before and sim_seconds > 0:
                rows.append(((sent - before) / sim_seconds, topic, node, connections))
    return sorted(rows, reverse=True)


def publish_rates(first, second, sim_seconds):
    """{(node, topic): messages published per sim second} from two snapshots ``sim_seconds`` apart: the growth of
    the count of each topic's oldest connection."""
    rates = {}
    for node, topics in second.items():
        for topic, (_, _, most) in topics.items():
            before = first.get(node, {}).get(topic, (0, 0, 0))[2]
            if sim_seconds > 0 and most > before:
                rates[(node, topic)] = (most - before) / sim_seconds
    return rates


def client_of(bus_stats):
    """'rospy' or 'roscpp' from the form of a node's getBusStats answer (published_counts reads both)."""
    return "rospy" if isinstance(bus_stats[0], int) else "roscpp"


def node_api(uri, timeout=NODE_TIMEOUT_S):
    """A node's XML-RPC API that gives up after ``timeout`` wall seconds (a node that hangs must not hang us)."""
    from landing_eval.isolated_ros import node_api as bounded_api
    return bounded_api(uri, timeout)


def snapshot(uris, caller="/bus_stats"):
    """{node: published_counts} of every node of ``uris`` ({node: XML-RPC URI}) that answers."""
    counts = {}
    for node, uri in uris.items():
        try:
            counts[node] = published_counts(node_api(uri).getBusStats(caller))
        except (OSError, xmlrpc.client.Error, IndexError, TypeError):  # gone, or an answer of another form
            pass
    return counts


def sim_seconds(snapshot_, clock_hz):
    """Sim seconds the simulator has run by a snapshot: the ticks of its oldest /clock connection."""
    return snapshot_.get(SIMULATOR, {}).get("/clock", (0, 0, 0))[2] / clock_hz
