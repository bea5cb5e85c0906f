# DRF's authtoken app (removed) kept operator tokens in plaintext; uninstalling the app leaves
# its table, and every old token in it, in the database and its backups. Drop it.
from django.db import migrations


class Migration(migrations.Migration):
    dependencies = [("operators", "0001_initial")]

    operations = [
        migrations.RunSQL(
            "DROP TABLE IF EXISTS authtoken_token", reverse_sql=migrations.RunSQL.noop
        ),
    ]
