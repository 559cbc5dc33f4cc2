from robocompose.grammar.rules import RULES, START_GRAPH, apply_rule, find_matches, first_match


def test_twenty_rules_in_reference_order():
    assert len(RULES) == 20
    assert [RULES[i].name for i in (0, 1, 2, 7, 10, 19)] == [
        "make_robot", "append_body", "make_body_with_legs", "end_head", "make_fixed_body_joint",
        "make_backwards_lift_limb_joint"]


def test_make_robot_builds_head_body_tail_chain():
    graph = apply_rule(RULES[0], START_GRAPH, first_match(RULES[0], START_GRAPH))
    assert [n.label for n in graph.nodes] == ["head", "body", "tail"]
    assert [(t, h, e.label) for t, h, e in graph.edges] == [(0, 1, "body_joint"), (1, 2, "body_joint")]


def test_first_match_is_lowest_parent_then_child():
    graph = apply_rule(RULES[0], START_GRAPH, (0,))
    # Two body_joint edges: head->body (0->1) and body->tail (1->2); the first match maps parent to node 0.
    matches = list(find_matches(RULES[10], graph))
    assert matches == [(0, 1), (1, 2)]
    assert first_match(RULES[10], graph) == (0, 1)


def test_matched_nodes_move_to_the_end_as_in_robogrammar():
    graph = apply_rule(RULES[0], START_GRAPH, (0,))
    fixed = apply_rule(RULES[10], graph, (0, 1))
    # head and body were matched: they follow the untouched tail, and the new fixed edge is last.
    assert [n.label for n in fixed.nodes] == ["tail", "head", "body"]
    assert fixed.edges[-1][2].joint_type == "fixed" and fixed.edges[-1][:2] == (1, 2)


def test_append_body_keeps_the_parent_edge_attributes():
    graph = apply_rule(RULES[0], START_GRAPH, (0,))
    graph = apply_rule(RULES[12], graph, first_match(RULES[12], graph))  # head->body becomes a swing hinge
    graph = apply_rule(RULES[1], graph, first_match(RULES[1], graph))
    labels = sorted(e.label or e.joint_type for _, _, e in graph.edges)
    assert labels == ["body_joint", "body_joint", "hinge"]


def test_end_rules_not_applicable_without_their_symbol():
    assert first_match(RULES[6], START_GRAPH) is None  # no tail yet
    assert first_match(RULES[5], START_GRAPH) is None  # no limb yet


def test_the_grammar_imports_no_physics_no_dataset_and_no_learning():
    from robocompose.io.provenance import PACKAGE_DIR, import_closure

    modules = [f"robocompose.grammar.{p.stem}" for p in (PACKAGE_DIR / "grammar").glob("*.py") if p.stem != "__init__"]
    used = {p.relative_to(PACKAGE_DIR).parts[0] for p in import_closure(*modules) if p.parent != PACKAGE_DIR}
    assert used <= {"grammar", "io"}, used  # io: the input-error class (io imports nothing of the project)
