"""``bayescal sensors``: the sensor cards (datasheet priors) bayescal knows."""


def add_parser(commands) -> None:
    parser = commands.add_parser("sensors", help="list the sensor cards (datasheet priors)")
    parser.set_defaults(run=run)


def run(args) -> int:
    from ..recording._sensor_cards import sensor_cards

    for card in sensor_cards():
        sections = [name for name in ("gyro", "accelerometer") if name in card.content]
        print(
            f"{card.name:<14} {card.content.get('grade', ''):<18} {'+'.join(sections):<20} "
            f"{card.datasheet}"
        )
    return 0
