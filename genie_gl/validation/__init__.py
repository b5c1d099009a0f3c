"""What a value must be, said the same way by the API and the command line: the words
(bounds), the API's argument checks (arguments) and the CLI's option types (options)."""
